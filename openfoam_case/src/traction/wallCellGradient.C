/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | TunnelQuake: water side, built against
   \\    /   O peration     | OpenFOAM v1912
    \\  /    A nd           |
     \\/     M anipulation  |
-------------------------------------------------------------------------------
License
    GPL-3.0-or-later, like the OpenFOAM libraries it links against.

\*---------------------------------------------------------------------------*/

#include "wallCellGradient.H"

// * * * * * * * * * * * * * * * * Local Functions * * * * * * * * * * * * * //

namespace
{

// The words of a scheme entry ("Gauss linear" -> (Gauss linear)); empty if
// it holds anything else
Foam::wordList schemeWords(Foam::ITstream& is)
{
    using namespace Foam;

    DynamicList<word> words;
    is.rewind();
    while (!is.eof())
    {
        token t(is);
        if (!t.good())
        {
            break;
        }
        if (!t.isWord())
        {
            is.rewind();
            return wordList();
        }
        words.append(t.wordToken());
    }
    is.rewind();
    return wordList(words);
}

} // End anonymous namespace


// * * * * * * * * * * * * * * * Global Functions  * * * * * * * * * * * * * //

bool Foam::tq::isGaussLinear(const fvMesh& mesh, const word& name)
{
    const wordList w(schemeWords(mesh.gradScheme(name)));
    return w.size() == 2 && w[0] == "Gauss" && w[1] == "linear";
}


bool Foam::tq::simpleDdtScheme
(
    const fvMesh& mesh,
    const word& name,
    bool& backward
)
{
    const wordList w(schemeWords(mesh.ddtScheme(name)));
    if (w.size() != 1)
    {
        return false;
    }
    backward = (w[0] == "backward");
    return backward || w[0] == "Euler";
}


// ************************************************************************* //
